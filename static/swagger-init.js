// Starts Swagger UI on /docs. An external file, not an inline script: the service's
// Content-Security-Policy (app/security.py) allows scripts from this server only.
(function () {
  const el = document.getElementById('swagger-ui');
  window.ui = SwaggerUIBundle({
    url: el.dataset.openapi,
    dom_id: '#swagger-ui',
    layout: 'BaseLayout',
    deepLinking: true,
    showExtensions: true,
    showCommonExtensions: true,
    presets: [SwaggerUIBundle.presets.apis, SwaggerUIBundle.SwaggerUIStandalonePreset],
  });
})();
